"""Identify: close the loop with measured data.

Planned (no code yet): compute the residual between a measurement (FRFs, cutting forces) and the
model, trace it to an effect the model lacks (a spindle mode, servo dynamics, a stiffness or
damping correction), add that effect as a :class:`linearize.Element`, refit, and report the error
before and after. It also holds ``robolobes study``, the comparison of the model with the paper's
measured facts.
"""
