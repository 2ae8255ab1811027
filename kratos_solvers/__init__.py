"""Every Kratos Multiphysics solver behind the component contract: the ALE fluid (``fluid``), the hyperelastic
solid (``solid``), the driver both share, which runs a Kratos analysis stage one coupling iteration at a time
(``stage``), ``.mdpa`` files (``mdpa``), and Mok's benchmark's fluid and structure (``mok``) with their meshes made by
gmsh (``mok_mesh``). Kratos and gmsh are imported only when a component is instantiated or a mesh is made: a scene
that names none of them needs neither."""
