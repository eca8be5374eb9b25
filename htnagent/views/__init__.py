"""A run for people to read: the live console trace, and a saved trace read back as a
history, a timeline picture, a map picture and an HTML report.  Built from trace events
alone; nothing below imports these."""
