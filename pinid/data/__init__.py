"""Recordings: the Dataset, file formats (a reader/writer registry), mapping specs, preprocessing.

The modules imported here register the built-in file formats (:mod:`pinid.data.registry`); a module
adding a format is imported here too, so that its reader is known wherever recordings are read.
"""

from pinid.data import csv_reader, npz_reader, mat_reader, formats, mapping, rosbag  # noqa: F401  (register the readers, writers)
