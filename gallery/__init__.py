"""The gallery's templates (``templates/``, Jinja2) and static files (``static/``).

Installed as the package data of ``inkmotion.gallery_assets``; the code that uses them is
:mod:`inkmotion.gallery`. A user's own templates (``inkmotion gallery build --templates
DIR``) replace these by name.
"""
