"""CLIP models (open_clip) for the image losses and the relevancy saliency: loading with honest
weights, augmentations, embeddings."""
