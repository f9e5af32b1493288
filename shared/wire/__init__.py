"""The wire: what crosses the services' HTTP boundary, and how each side is configured.

Pydantic schemas of both APIs, error bodies, request-body limits, access control, settings, the
Python clients of both services and the paper's pySpatial API on top of them. Builds on
`geometry`, `imaging` and `questions`; never on `services`.
"""
