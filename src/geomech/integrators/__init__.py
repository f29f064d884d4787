"""Simulation: integrators and exact propagation."""

from .quadrature import CriticalPoint, OrbitIntegral, QuadraturePropagator, SerretAndoyerPropagator

__all__ = ["CriticalPoint", "OrbitIntegral", "QuadraturePropagator", "SerretAndoyerPropagator"]
