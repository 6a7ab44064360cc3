"""The FFR discontinuous-beam model (Koda et al. 2025): scene -> mesh -> 12-DOF Euler-Bernoulli beam
elements -> assembly -> modes -> point kinematics -> moving-base dynamics (FFRBeam.fmu's simulator)."""
