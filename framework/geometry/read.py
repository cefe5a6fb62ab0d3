"""Old home of :func:`read_input` and :func:`is_scheme`, kept importable while the last
importer (``plugins/fit.py``) moves to :mod:`inkmotion.kinds.read` and
:mod:`inkmotion.inputs.sources` (issue 21); to be deleted then. Nothing new imports it."""

from inkmotion.inputs.sources import is_scheme
from inkmotion.kinds.read import read_input

__all__ = ["is_scheme", "read_input"]
