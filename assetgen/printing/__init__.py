"""What helps printed parts fit: the clearance gauge (assetgen/printing/gauge.py)."""
