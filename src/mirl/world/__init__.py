"""The world model (second layer from the bottom): what the robots are and where — grid maps
(text, ROS ``map_server``, generated offices) and their metric frame, the patrol domain (states,
ψ, ξ, φ, detection), the motion model of Eq. 5, the interaction game and scenarios.

It is static description, nothing here runs or learns; it may import only :mod:`mirl.mdp`.
"""
