"""The Thicket node editor (issue 17): `tree` (the node tree, socket, nodes, add
menu and sidebar panel), `graph` (a node tree read into a field tree's JSON, handle
objects resolved) and `live` (Field Mesh objects linked to a tree, regenerated when
it or a handle changes)."""
