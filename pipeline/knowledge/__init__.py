"""The ontology and RDF: the vocabulary, the population of individuals, reasoning, SHACL, export."""
