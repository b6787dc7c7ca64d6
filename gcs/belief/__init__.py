"""What the GCS believes between reports, as pure models: each aMussel's duty (drain and wake schedule), a
simulated aMussel's battery run forward from its last report, a real one's estimate, the aPad's energy budget."""
