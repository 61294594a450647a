"""`python -m sweep.cli ...`: the program, as `python -m sweep` and the `sweep` command run it."""
from ..program import main

main()
