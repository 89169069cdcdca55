"""Observations (data types): what L recorded of the robots — grid trajectories
``t,robot,row,col,heading`` with their CSV reader and writer (:mod:`.trajectories`), continuous
pose tracks ``t,robot,x,y,yaw`` from CSV (:mod:`.poses`) and ROS bags / MCAP (:mod:`.bags`),
their discretisation onto a scenario's grid (:mod:`.discretise`), and one loader for any of
these files (:mod:`.sources`).

Algorithms take these records, worlds produce them; this stage may import only
:mod:`mirl.world` and :mod:`mirl.mdp`.
"""
