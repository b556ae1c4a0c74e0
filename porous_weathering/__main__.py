from porous_weathering.cli.entry import exit_with

exit_with()
