"""The runtime wing: what makes a run start fast and reproducibly on any machine, apart from
what it computes (`xla.py`: XLA's flags, the compilation cache, devices started early).
"""
