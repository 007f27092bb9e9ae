"""Live components (docs/ros.md): a program subscribed to topics, publishing what its
subscribers asked for, answering service calls.

- `config`: the pub_sub.xml of thesis Listing 2.2.
- `node`: `LiveNode`, shared by every middleware: one consumer thread feeds the Engine in
  arrival order; the services of thesis A.1.
- `ros1`, `ros1_services`: ROS 1 through Debian's rospy (`retalisc ros`).
"""
