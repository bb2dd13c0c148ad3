"""Families of assemblies: parameters, a sampler, and a pure function to parts and steps."""
