"""Reports: results as JSON, Markdown and a self-contained HTML page with plots (matplotlib, Agg)."""
