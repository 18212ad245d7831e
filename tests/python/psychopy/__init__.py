"""A stand-in for the `psychopy` package, for tests/instrument/psychopy_clients.rs.

psychopy-photoresearch (PsychoPy's Photo Research clients, PyPI) imports only
`psychopy.logging` from PsychoPy itself; installing all of PsychoPy for that
would pull in a GUI stack. This package provides that one module and nothing
else: the clients' own code runs unchanged.
"""
