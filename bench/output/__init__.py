"""Reports (tables, HTML) and figures."""
