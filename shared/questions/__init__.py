"""Questions: multiple-choice options, answer letters, and the typed intent of a spatial question.

Text in, typed records out. Uses the motion vocabulary of `shared.geometry`, nothing else.
"""
