"""The `contact-bench` command line."""
