"""The planning model: terms, beliefs, operators and methods, ground actions, plans as values.

Plain synchronous values that check themselves when built; nothing here searches or runs.
"""
