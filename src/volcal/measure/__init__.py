"""Laser reading models and the virtual machine that simulates every test."""
