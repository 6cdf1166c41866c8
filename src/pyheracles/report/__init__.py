"""Reports: pictures and tables of results."""
