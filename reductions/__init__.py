"""Reductions from the finite-element beam to lower fidelities (paper Eqs. 42-46)."""
