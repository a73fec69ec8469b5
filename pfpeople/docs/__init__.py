"""Documentation generated from the code: the configuration reference (:mod:`pfpeople.docs.reference`).

Its own folder because it reads every part a configuration names (the schema, the detectors' constructors, the
tracker's and the clutter map's settings) and nothing imports it back.
"""
