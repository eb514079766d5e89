"""Example sweep files (``*.toml``) for ``spurdiff sweep``; see docs/sweeps.md."""
