"""Recordings: the Dataset, file formats, mapping specs, preprocessing."""
