"""The elastic tube (the paper's first example): its report plot and its stability matrix."""
