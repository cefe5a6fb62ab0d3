"""Readers' algorithms: GML/JSON tags, SVG paths and Hershey text parsed into traces
(the reader plugins wrap them)."""
