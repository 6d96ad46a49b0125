"""Time-integration / contact schemes, one module each (see `contact_bench.api.registry`)."""
