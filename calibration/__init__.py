"""Calibration of warpdem models with a genetic algorithm over batched worlds (see the calibration issue)."""
