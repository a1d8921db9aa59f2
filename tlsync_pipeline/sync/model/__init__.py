"""Shared types and the configuration's leaves: parameters, declared methods, camera clock, status, log error model."""
