"""Cameras, rendering and point clouds."""
