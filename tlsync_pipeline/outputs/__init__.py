"""What a run gives people and other tools: exports, pictures, plots and report text, as
functions of typed values (the pipeline's stages write them through the Workspace)."""
