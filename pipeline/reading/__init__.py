"""Reading a robot description: the URDF (hardened), xacro in a sandbox, the kinematic tree and what the file says of each link."""
