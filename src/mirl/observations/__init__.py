"""Observations (data types): what L recorded of the robots — grid trajectories
``t,robot,row,col,heading`` with their CSV reader and writer.

Algorithms take these records, worlds produce them; this stage may import only
:mod:`mirl.world` and :mod:`mirl.mdp`.
"""
