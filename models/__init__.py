"""Model assets and generators: arm, table, tools, rack, skull phantom, parts, user meshes."""
