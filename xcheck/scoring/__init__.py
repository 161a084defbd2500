"""Scoring any simulator's output (issue 39): a trajectory file read by its declared conventions
(:mod:`.convention`, :mod:`.reader`), scored against a scenario's reference (:mod:`.score`), the usual convention
mistakes tried when it fails (:mod:`.detective`), and the local NED frame of a rotating Earth that flight simulators
report attitudes in (:mod:`.earth`)."""
