"""cosim's libprecice: preCICE v3's C++, C and Fortran APIs served by cosim's coupler (the C++ sources here, built
and installed by ``cosim libprecice install``; ``build`` finds and builds it)."""
