"""Time-integration / contact schemes, one module each (see `bench.registry`)."""
