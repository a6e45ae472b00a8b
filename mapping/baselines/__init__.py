"""The clusterings a user would put beside the manifold method.

Normalised cut with the best kernel width in hindsight and self-tuning spectral clustering
(``spectral``; the paper's
comparisons), the label-free choices of the eigengap and scikit-learn's k-NN spectral
clustering (``label_free``), and the sweep over kernel widths (``sigma_sweep``).
"""

from common.lazy import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    {
        "EigengapNCutClustering": "mapping.baselines.label_free",
        "KNNSpectralClustering": "mapping.baselines.label_free",
        "NormalizedCutClustering": "mapping.baselines.spectral",
        "SelfTuningSpectralClustering": "mapping.baselines.spectral",
        "SigmaSweep": "mapping.baselines.sigma_sweep",
        "best_sigma_ncut": "mapping.baselines.sigma_sweep",
        "default_sigmas": "mapping.baselines.sigma_sweep",
        "eigengap": "mapping.baselines.label_free",
    },
)
