"""Reports: results as JSON, Markdown and an HTML page with its plots beside it (matplotlib, Agg)."""
