from porous_weathering.cli import exit_with

exit_with()
