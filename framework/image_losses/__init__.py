"""image_losses"""
