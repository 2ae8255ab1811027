"""Two Kratos CoSimulation cases in Kratos's own file layout, on the Mok channel's generated meshes: a static wall
and a dynamic one (``cases.kratos_wall.write``)."""
