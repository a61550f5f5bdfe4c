"""The scenario language: a YAML file's text to a validated :class:`~stackdsl.lang.schema.Scenario`
(or a sweep's template), every error at its file:line:col. The ground floor of stackdsl.

Source: stackdsl's own.
"""
