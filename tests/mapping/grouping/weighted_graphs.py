"""Small weighted graphs the grouping tests share."""

import numpy as np

# a weighted graph whose normalized and unnormalized bisections differ
UNEVEN = np.array(
    [
        [0.0, 0.0, 0.0, 0.0, 0.8, 0.9],
        [0.0, 0.0, 0.5, 0.0, 0.8, 0.0],
        [0.0, 0.5, 0.0, 0.2, 0.0, 0.5],
        [0.0, 0.0, 0.2, 0.0, 0.7, 0.6],
        [0.8, 0.8, 0.0, 0.7, 0.0, 0.0],
        [0.9, 0.0, 0.5, 0.6, 0.0, 0.0],
    ]
)
