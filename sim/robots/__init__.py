"""Robots that hold the peg in place of the floating peg's velocity actuators."""
