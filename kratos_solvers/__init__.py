"""The Kratos Multiphysics solvers behind the component contract: the ALE fluid (``fluid``), the hyperelastic
solid (``solid``) and the driver both share, which runs a Kratos analysis stage one coupling iteration at a time
(``stage``). Kratos is imported only when a component is instantiated: a scene that names none of them needs none of
Kratos."""
