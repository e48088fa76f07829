"""Input and output: the files vibeam reads (measured FRCs, tables) and the one results writer
(netCDF4/CF in HDF5), with the output folder's locking and atomic replacement."""
