"""``rlchain compare``: run folders -> reward (and success rate, ``env_info/*``) against frames and seconds
with seed bands (PNG) and a Markdown table of IQM with bootstrap confidence intervals.

``runs`` reads the TensorBoard events of run folders, ``stats`` holds the statistics (IQM, stratified
bootstrap), ``report`` the table, ``plot`` the figures (matplotlib, imported only when drawing), ``cli`` the command.
"""
