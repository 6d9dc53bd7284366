"""Markdown/HTML reports and figures (matplotlib is imported inside the drawing functions)."""
