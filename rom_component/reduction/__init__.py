"""The reduction both ROM families share: POD, encoders, decoders, the quadratic manifold."""
