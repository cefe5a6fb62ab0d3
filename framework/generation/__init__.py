"""CLIP-driven generation: the shared machinery of the 'tag' and 'abstract' job kinds."""
