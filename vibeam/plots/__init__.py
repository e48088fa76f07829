"""Figures: the house style and the sweep figures (FRC, bifurcation diagram)."""
