"""plant_rt."""
