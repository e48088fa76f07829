"""The engine: the one sweep engine and its executors, the runner of a case, per-point outputs
(records), scene effects and the sensor, and the compile clock."""
