"""`python -m sweep ...`: the same program as the `sweep` console script."""
from .program import main

main()
