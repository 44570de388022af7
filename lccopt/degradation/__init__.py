"""Track degradation over many axle passes: settlement laws and the block iteration that
couples them to the vehicle-track simulation (docs/settlement.md)."""
