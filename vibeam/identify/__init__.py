"""Identification: the rig's linear parameters and fits of model parameters to measured FRCs."""
