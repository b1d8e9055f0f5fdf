"""pmpm: MPI-parallel material point method for impact and penetration."""
__version__ = "0.1.0"
