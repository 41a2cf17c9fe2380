"""Simulated execution in MuJoCo: does the exported trajectory put the object down?"""
