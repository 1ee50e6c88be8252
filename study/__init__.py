"""The study: the TX200 model beside the paper's measured facts (``robolobes study``)."""
