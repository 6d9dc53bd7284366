"""Recordings: the Dataset, file formats (a reader/writer registry), mapping specs, preprocessing.

The modules imported here register the built-in file formats (:mod:`pinid.data.registry`); a module
adding a format is imported here too, so that its reader is known wherever recordings are read.
"""

from pinid.data import formats, mapping  # noqa: F401  (register the CSV and NPZ readers and writers)
