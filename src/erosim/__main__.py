"""`python -m erosim …` runs the command-line program, the same as `erosim …`."""

from erosim.cli import main

main()
