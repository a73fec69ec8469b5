"""The bag pipeline: sensor setup, the front end, the filter, classifier and tracker built from the
configuration, the run loop, mounts followed over TF, and many bags on Dask."""
