"""lccopt: level-crossing design optimisation with a vehicle-track interaction model."""
__version__ = "0.1.0"
