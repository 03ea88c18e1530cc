"""unseeable: estimate Lincoln Log assemblies, including the logs a camera cannot see.

Implements and extends Narayanaswamy, Barbu & Siskind, "Seeing Unseeability
to See the Unseeable". The pipeline stages are subpackages: :mod:`.domain`,
:mod:`.grammar`, :mod:`.solve`, :mod:`.camera`, :mod:`.render`, :mod:`.vision`,
:mod:`.visibility`, :mod:`.confidence`, :mod:`.corpus`, :mod:`.evaluate`,
:mod:`.cli`.
"""

from unseeable.errors import InputError, SolverError, UnseeableError

__version__ = "0.1.0"

__all__ = ["UnseeableError", "InputError", "SolverError", "__version__"]
