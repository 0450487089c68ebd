"""What drives the wheels: DC motors (WPILib's model, SysId gains), a robot's dynamics
(mass, battery, traction), the rigid-body force map, and the motor-aware limit rows,
NLP constraints and clamp step built from them."""
