"""Literate demos; each module registers one scene (see pyproject.toml, entry points rodfem.scenes)."""
