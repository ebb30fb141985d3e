"""A swarm closed to all but its members: Zenoh's mutual TLS and access control.

``pki`` makes certificates, ``acl`` the router's rules, ``configs`` the JSON5 configs,
``deploy`` a swarm's directory, ``checks`` the TLS files a config names.
"""
