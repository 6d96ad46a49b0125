"""Scenes (cases), one module each (see `contact_bench.api.registry`)."""
