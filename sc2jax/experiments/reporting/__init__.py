"""What runs report: the CSV log and progress bar, TensorBoard events, learning-curve
plots, markdown sections, and the paper's Table 1 to compare with."""
