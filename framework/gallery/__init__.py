"""The gallery: a static website of every job, built from the job store and results folders.

``inkmotion gallery build`` = :func:`~inkmotion.gallery.entries.collect` (what to show) then
:func:`~inkmotion.gallery.build.build_gallery` (Jinja2 templates from the project's
``gallery/templates``, pages written atomically and incrementally). Importing this package
imports no torch.
"""

from inkmotion.gallery.build import BuildReport, build_gallery
from inkmotion.gallery.entries import Entry, collect, from_folder, from_record

__all__ = ["BuildReport", "Entry", "build_gallery", "collect", "from_folder", "from_record"]
