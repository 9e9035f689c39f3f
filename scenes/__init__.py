"""The example and benchmark scenes with their textures and meshes, shipped inside the
wheel as the package ``texray.scenes`` (``texray bench`` finds its suite here)."""
