"""Scenes (cases), one module each (see `bench.registry`)."""
