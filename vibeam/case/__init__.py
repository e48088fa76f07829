"""Case files: the schema of a scene (TOML, pydantic), its text, contact laws, the arguments of the
command line and API checked by the same rules, and beam scenes (FE model and SDOF reduction)."""
