"""Output and input files: the XDMF series for ParaView, ``anchors.csv``, the JSON summary,
checkpoints, the output folder and its lock."""
