"""How robots are described: the wheel-type registry, robot files and presets (TOML),
the mobility analysis of wheel sets, wheel sets by type, and other sources' wheel
conventions."""
