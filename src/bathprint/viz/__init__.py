"""Pictures of the filament: static figures and the interactive 3D viewer."""
