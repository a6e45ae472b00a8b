"""Features both mapping methods cluster.

Images as vectors (``images``) or as per-cell HSV colour histograms (``hsv_histograms``), laser
scans as range vectors (``scans``) and as rotation-invariant statistics (``statistics``). Each
is a scikit-learn transformer.
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "IMAGE_NORMALIZATIONS": "mapping.features.images",
        "ColorHistogramFeatures": "mapping.features.hsv_histograms",
        "ImageFeatures": "mapping.features.images",
        "color_histograms": "mapping.features.hsv_histograms",
        "images_to_vectors": "mapping.features.images",
        "normalize_rows": "mapping.features.images",
        "SCAN_REPRESENTATIONS": "mapping.features.scans",
        "ScanFeatures": "mapping.features.scans",
        "ScanRangesInput": "mapping.features.scans",
        "scan_ranges": "mapping.features.scans",
        "scan_vectors": "mapping.features.scans",
        "SCAN_STATISTICS": "mapping.features.statistics",
        "ScanStatistics": "mapping.features.statistics",
        "scan_statistics": "mapping.features.statistics",
    },
)
