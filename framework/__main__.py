"""``python -m inkmotion`` runs the command line."""

from inkmotion.cli.main import main

main()
