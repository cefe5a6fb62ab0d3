"""The picture files a drawing may be given as: one home for their suffixes and for how
help texts and refusals name them. No imports: the CLI reads this to write its help."""

from __future__ import annotations

#: file suffixes read as pictures (HEIC/HEIF only with the pillow-heif plugin installed;
#: without it such a photo is refused in one sentence saying what to do; a PDF, which a
#: scanner often writes, is refused with how to export its page as a picture)
PICTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp", ".gif",
                    ".pgm", ".ppm", ".avif", ".jp2", ".heic", ".heif", ".pdf")
#: the picture formats as a user knows them, for help texts and refusals
PICTURE_FORMATS = "PNG, JPEG, BMP, TIFF, WebP, AVIF, GIF, JPEG 2000, PGM/PPM"
