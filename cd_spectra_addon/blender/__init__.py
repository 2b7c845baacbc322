"""The Blender layer: everything that imports bpy (operators, panels, light builders, decoders)."""
