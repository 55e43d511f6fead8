"""Measuring motion: foot contacts, foot skating, cadence, jerk, reconstruction errors."""
