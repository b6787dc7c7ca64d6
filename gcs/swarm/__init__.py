"""Several aPads sharing one fleet: the split (k-means, balanced: `partition`), who serves and who holds
whom, re-sharing when an aPad is lost or back, and legs kept apart (`shares`)."""
