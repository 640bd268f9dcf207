"""What a deployment needs besides the code: the robot-info YAMLs (`robots/`) and an example
site configuration, shipped as package data so an installed runtime finds them."""
