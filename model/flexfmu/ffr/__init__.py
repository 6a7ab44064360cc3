"""The FFR discontinuous-beam model (Koda et al. 2025): scene -> mesh -> 12-DOF beam elements (flexfmu.ffr.elements:
Euler-Bernoulli, Timoshenko) -> assembly -> modes -> point kinematics -> moving-base dynamics (FFRBeam.fmu's
simulator)."""
