"""Analysis of results: runs grouped into cells, the sweep report with the thesis's claims, contact analysis."""
