"""The drop model: a ball released from rest, bouncing on a floor, as measurements see it.

``simulate``: the event-driven simulator (closed-form flights, exact impacts, many drops in one
vectorised call) and what an experimenter would record of a drop. ``effects``: the registry of
candidate effects the paper's constant-ε model leaves out (air drag, a speed-dependent ε,
contact duration, a tracked point that is not the bottom, buoyancy), shared by the simulator and
the fitter. ``synthetic``: drop tests with hidden effects, the test cases of discovery.

Builds on :mod:`vrcal.model`; :mod:`vrcal.discovery` builds on it.
"""
